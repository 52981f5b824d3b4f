"""The ``--html`` report in a real browser (headless Chromium, driven by Playwright, every
request that is not the file itself refused): it opens with no console error, draws the part
and the time series, hover names a block's line, a click on a table row zooms both views to
the block; ``k37 effects --html`` likewise. Without Chromium or Playwright these skip, saying
so. The data the page carries (levels that keep every peak, the blocks' N-words) are checked
without a browser."""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np
import pytest

from k37.firmware_model.job import MachineConfig
from k37.sim.cli import main
from k37.sim.run.output import summary
from k37.sim.run.plot_data import PlotData
from k37.sim.run.report_html.page import packed
from k37.sim.run.report_html.run_page import run_page
from k37.sim.run.report_html.series import COARSEST, MERGE, levels
from k37.sim.run.runner import RunOptions, run_job
from tests.paths import ROOT
from tests.programs import surface_finish

CHROMIUM = Path("/usr/bin/chromium")
#: Chromium's switches for a test: headless, no sandbox (root in CI), nothing fetched.
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
SQUARE = ROOT / "examples" / "square.ngc"


@pytest.fixture(scope="module")
def browser():
    if not CHROMIUM.exists():
        pytest.skip(f"no browser: {CHROMIUM} is not installed (Debian: apt-get install "
                    f"chromium)")
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="no Playwright: pip install -e '.[test]'")
    with sync_api.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        yield chromium
        chromium.close()


class Opened:
    """A page opened from a file, with every console error and every request elsewhere."""

    def __init__(self, browser, path: Path):
        self.errors: list[str] = []
        self.elsewhere: list[str] = []
        self.page = browser.new_page(viewport={"width": 1400, "height": 1000})
        self.page.on("console", lambda m: m.type == "error" and self.errors.append(m.text))
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))

        def route(r):
            if r.request.url.startswith("file:"):
                r.continue_()
            else:
                self.elsewhere.append(r.request.url)
                r.abort()

        self.page.route("**/*", route)
        self.page.goto(path.as_uri())
        self.page.wait_for_function("window.Plotly !== undefined")

    def value(self, script: str):
        return self.page.evaluate(script)


@pytest.fixture(scope="module")
def square(tmp_path_factory) -> Path:
    """``examples/square.ngc``'s report (its blocks numbered N20 ... N70)."""
    out = tmp_path_factory.mktemp("html") / "square.html"
    assert main(["run", str(SQUARE), "--html", str(out), "-q"]) == 0
    return out


def test_the_page_is_one_file_that_fetches_nothing(square):
    text = square.read_text()
    assert not re.search(r"<(script|link)[^>]+(src|href)=", text)
    assert "Plotly" in text and "k37-data" in text


def test_the_report_opens_without_console_errors_and_draws_part_and_series(browser, square):
    opened = Opened(browser, square)
    page = opened.page
    page.wait_for_selector("#part .main-svg")
    page.wait_for_selector("#series .main-svg")
    assert opened.value("document.getElementById('part').data.length") == 4
    drawn = opened.value("document.getElementById('series').data.map(t => t.x.length)")
    assert len(drawn) >= 8 and min(drawn) > 10  # every series has points
    assert page.locator("#series .scatterlayer .trace").count() == len(drawn)
    rows = page.locator("#blocks tbody tr")
    assert rows.count() == 6
    assert page.locator("#blocks tbody tr td:first-child").all_inner_texts() == [
        f"N{n}" for n in range(20, 80, 10)]
    assert "max" in page.locator("#summary").inner_text()
    assert not opened.errors and not opened.elsewhere


def test_hovering_the_part_names_the_blocks_line(browser, square):
    opened = Opened(browser, square)
    page = opened.page
    page.wait_for_selector("#part .main-svg")
    # the middle of the third block's actual path, in the page's pixels
    x, y = opened.value("""(() => {
        const gd = document.getElementById('part');
        const trace = gd.data[1], rows = [];
        for (let i = 0; i < trace.customdata.length; i++)
            if (trace.customdata[i][0] === 'N40') rows.push(i);
        const i = rows[rows.length >> 1];
        const full = gd._fullLayout, box = gd.getBoundingClientRect();
        return [box.left + full._size.l + full.xaxis.l2p(trace.x[i]),
                box.top + full._size.t + full.yaxis.l2p(trace.y[i])];
    })()""")
    page.mouse.move(x, y)
    label = page.locator("#part .hoverlayer .hovertext")
    label.wait_for()
    text = label.text_content()
    assert "N40" in text and "line 6" in text and "feed 900.0 mm/min" in text
    assert not opened.errors


def test_hovering_a_time_marks_the_tools_place_on_the_part(browser, square):
    opened = Opened(browser, square)
    page = opened.page
    page.wait_for_selector("#series .main-svg")
    page.locator("#series").scroll_into_view_if_needed()
    box = page.locator("#series").bounding_box()
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + 200)
    page.locator("#series .hoverlayer .hovertext").first.wait_for()
    page.wait_for_function("document.getElementById('part').data[3].x.length === 1")
    # the marker is the actual position at the first sample from the time hovered
    marker, sample = opened.value("""(() => {
        const t = document.getElementById('series')._hoverdata[0].x;
        const time = unpack(K37.series.time);
        let i = 0;
        while (i < time.length - 1 && time[i] < t) i++;
        const part = document.getElementById('part').data[3];
        return [[part.x[0], part.y[0]], [unpack(K37.actual.x)[i], unpack(K37.actual.y)[i]]];
    })()""")
    assert marker == sample and sample != [0, 0]
    assert not opened.errors


def test_a_click_on_a_row_zooms_both_views_to_its_block(browser, square):
    opened = Opened(browser, square)
    page = opened.page
    page.wait_for_selector("#series .main-svg")
    whole = opened.value("document.getElementById('series').layout.xaxis.range")
    # 18,528 samples: the whole run drawn from a coarser level, a block from a finer one
    level = opened.value("window.k37Report.view().level")
    assert level > 0
    page.locator("#blocks tbody tr", has_text="N50").click()
    page.wait_for_function("document.getElementById('part').layout.xaxis.range !== undefined"
                           " && !document.getElementById('part').layout.xaxis.autorange")
    start, end = opened.value("(() => { const k = K37.blocks.label.indexOf('N50');"
                              " return [K37.blocks.start[k], K37.blocks.end[k]]; })()")
    t0, t1 = opened.value("document.getElementById('series').layout.xaxis.range")
    assert t0 < start < end < t1 and t1 - t0 < (end - start) * 1.5 < whole[1] - whole[0]
    # the part: the view centred on the block (from (12, 12) to (2, 12) mm; the whole
    # square's centre is (7, 7)), its height a little more than the block's length
    x0, x1 = opened.value("document.getElementById('part').layout.xaxis.range")
    y0, y1 = opened.value("document.getElementById('part').layout.yaxis.range")
    assert x0 < 2 and x1 > 12 and (x0 + x1) / 2 == pytest.approx(7, abs=0.1)
    assert (y0 + y1) / 2 == pytest.approx(12, abs=0.1) and 10 < y1 - y0 < 13
    assert page.locator("#blocks tbody tr.selected").inner_text().startswith("N50")
    assert opened.value("window.k37Report.view().level") < level
    assert not opened.errors


def test_a_click_on_a_heading_sorts_the_blocks(browser, square):
    opened = Opened(browser, square)
    page = opened.page
    page.locator("#blocks th", has_text="max contour error").click()
    page.locator("#blocks th", has_text="max contour error").click()  # largest first
    first = page.locator("#blocks tbody tr").first.locator("td").nth(9).inner_text()
    assert float(first) == pytest.approx(max(opened.value("K37.blocks.max")), abs=0.006)


def test_the_study_page_links_its_runs_and_draws_the_effects(browser, tmp_path):
    rows = ["run,kp,tm,status,circularity"] + [
        f"{k},{kp},{tm},ok,{1 + kp / 10 + tm * 100 + (kp / 10) ** 2}"
        for k, (kp, tm) in enumerate([(a, b) for a in (10, 20, 30) for b in (0.01, 0.02, 0.03)])]
    (tmp_path / "results.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "3.html").write_text("<html></html>")
    assert main(["effects", str(tmp_path), "--metric", "circularity", "--html"]) == 0
    opened = Opened(browser, tmp_path / "effects_circularity.html")
    opened.page.wait_for_selector("#surface .main-svg")
    assert opened.value("document.getElementById('effects').data.length") == 2
    links = opened.page.locator("#runs a")
    assert links.count() == 1 and links.first.get_attribute("href") == "runs/3.html"
    assert not opened.errors and not opened.elsewhere


def test_every_level_keeps_the_peaks_and_the_coarsest_is_small():
    n = 200_000
    values = np.zeros((n, 4))
    values[:, 0] = np.arange(n) * 1000
    values[123_457, 3] = 7.5  # one spike
    values[7, 3] = -2.0
    data = PlotData(("cycle", "x_actual", "y_actual", "x_error"), 1, values, values, values,
                    [], n)
    lv = levels(data, MachineConfig(), 1e6, ["x_error", "path_speed"])
    assert len(lv.low["x_error"]) > 3
    for low, high in zip(lv.low["x_error"], lv.high["x_error"], strict=True):
        assert high.max() == 7.5 and low.min() == -2.0
    assert len(lv.low["x_error"][-1]) <= COARSEST
    sizes = [len(level) for level in lv.low["x_error"]]
    assert all(a == -(-b // MERGE) for a, b in zip(sizes[1:], sizes, strict=False))


def test_packed_arrays_are_little_endian_base64():
    p = packed([1.5, -2.0])
    assert p["dtype"] == "f4"
    assert np.frombuffer(base64.b64decode(p["b64"]), "<f4").tolist() == [1.5, -2.0]


def test_the_page_carries_every_blocks_line_and_the_reports_max(make_job):
    result = run_job(make_job("N5 G21 G90 F1200\nG01 X3\nN30 G01 Y2\nM30", name="lines"),
                     RunOptions(sample_every=500))
    text = run_page(result, summary(result))
    data = json.loads(re.search(r'id="k37-data" type="application/json">(.*?)</script>',
                                text).group(1))
    assert data["blocks"]["line"] == [b["line"] for b in result.report["blocks"]]
    assert data["blocks"]["label"] == ["line 2", "N30"]
    assert max(data["blocks"]["max"]) == pytest.approx(
        result.report["path"]["max_contour_error"], rel=1e-6)


@pytest.mark.slow
def test_a_3d_cam_program_of_3000_blocks_opens_with_every_line_and_the_max(browser, tmp_path):
    program = tmp_path / "surface.ngc"
    program.write_text(surface_finish() + "\n")
    job = tmp_path / "surface.toml"
    job.write_text('name = "surface"\n[machine]\naxes = 3\naccel = "post"\naccel_bits = 10\n'
                   '[program]\nfile = "surface.ngc"\n')
    page, report = tmp_path / "surface.html", tmp_path / "surface.json"
    assert main(["run", str(job), "--html", str(page), "--json", str(report), "-q"]) == 0
    report = json.loads(report.read_text())
    assert len(report["blocks"]) > 3000
    opened = Opened(browser, page)
    opened.page.wait_for_selector("#part .gl-container canvas")
    opened.page.wait_for_selector("#series .main-svg")
    assert opened.value("document.getElementById('part').data[1].type") == "scatter3d"
    lines = opened.value("K37.blocks.line")
    assert lines == [b["line"] for b in report["blocks"]]
    assert opened.page.locator("#blocks tbody tr").count() == len(lines)
    assert max(opened.value("K37.blocks.max")) == pytest.approx(
        report["path"]["max_contour_error"], rel=1e-6)
    assert f"{report['path']['max_contour_error']:.2f} LSB" in opened.page.locator(
        "#summary").inner_text()
    assert not opened.errors and not opened.elsewhere


def test_a_ballbar_run_shows_its_polar_plot(browser, tmp_path):
    circle = ROOT / "examples" / "circle.toml"
    page = tmp_path / "circle.html"
    assert main(["run", str(circle), "--ballbar", str(tmp_path / "bb.png"), "--html",
                 str(page), "-q"]) == 0
    opened = Opened(browser, page)
    opened.page.wait_for_selector("#ballbar .main-svg")
    assert opened.page.locator("#ballbar-section").is_visible()
    measured = opened.value("document.getElementById('ballbar').data[1].r.length")
    assert measured > 100
    assert "circularity" in opened.page.locator("#ballbar .gtitle").text_content()
    assert not opened.errors


@pytest.mark.slow
def test_a_sweep_writes_each_runs_report_and_the_study_page_links_them(browser, tmp_path):
    (tmp_path / "base.toml").write_text(
        '[machine]\naccel = "none"\n[program]\ngcode = """\nG21 G90 F{feed}\n'
        'G03 X0 Y0 I-{radius} J0\nM30\n"""\n')
    (tmp_path / "study.toml").write_text(
        'base = "base.toml"\ndesign = "grid"\n[factors]\nfeed = [600, 1200]\nradius = [1]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(tmp_path / "study.toml"), "--out", str(out), "--html", "-j", "1",
                 "-q"]) == 0
    assert sorted(p.name for p in (out / "runs").iterdir()) == ["0.html", "1.html"]
    assert main(["effects", str(out), "--metric", "max_contour_error", "--html"]) == 0
    opened = Opened(browser, out / "effects_max_contour_error.html")
    links = opened.page.locator("#runs a")
    assert [links.nth(k).get_attribute("href") for k in range(links.count())] == [
        "runs/0.html", "runs/1.html"]
    links.nth(1).click()
    opened.page.wait_for_selector("#ballbar .main-svg")  # a circle: its ballbar too
    assert opened.page.url.endswith("runs/1.html")
    assert not opened.errors and not opened.elsewhere


def test_a_job_name_with_markup_stays_text(make_job):
    result = run_job(make_job("G21 G90 F1200\nG01 X1\nM30", name="</script><b>x&y"),
                     RunOptions(sample_every=500))
    text = run_page(result, summary(result))
    assert text.count("</script>") == text.count("<script") == 4
    assert "<b>x" not in text and "&lt;/script&gt;&lt;b&gt;x&amp;y" in text

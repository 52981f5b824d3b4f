"""A screenshot of an ``--html`` report, as the docs show it: the page opened in headless
Chromium (Debian's ``chromium``, through Playwright; nothing fetched), a point of the part
hovered, the whole page saved as PNG.

Run with ``python bench/html_screenshot.py REPORT.html OUT.png [LABEL]`` (LABEL: the block
whose middle is hovered, default ``N40``); the docs' picture is of ``examples/square.ngc``::

    k37 run examples/square.ngc --html square.html -q
    python bench/html_screenshot.py square.html docs/tutorial/square_html.png
"""

from __future__ import annotations

import sys
from pathlib import Path

from playwright.sync_api import sync_playwright

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
#: The script that finds the middle of a block's actual path, in the page's pixels.
HOVER = """(label) => {
    const gd = document.getElementById('part');
    const trace = gd.data[1], rows = [];
    for (let i = 0; i < trace.customdata.length; i++)
        if (trace.customdata[i][0] === label) rows.push(i);
    const i = rows[rows.length >> 1];
    const full = gd._fullLayout, box = gd.getBoundingClientRect();
    return [box.left + full._size.l + full.xaxis.l2p(trace.x[i]),
            box.top + full._size.t + full.yaxis.l2p(trace.y[i])];
}"""


def screenshot(report: Path, out: Path, label: str = "N40") -> None:
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
        page = browser.new_page(viewport={"width": 1300, "height": 900})
        page.route("**/*", lambda r: r.continue_() if r.request.url.startswith("file:")
                   else r.abort())
        page.goto(report.resolve().as_uri())
        page.wait_for_selector("#series .main-svg")
        page.mouse.move(*page.evaluate(HOVER, label))
        page.wait_for_selector("#part .hoverlayer .hovertext")
        page.screenshot(path=str(out), full_page=True)
        browser.close()


if __name__ == "__main__":
    screenshot(Path(sys.argv[1]), Path(sys.argv[2]), *sys.argv[3:4])

"""Run a job from Python and read its report and traces as numpy arrays.

    python examples/api_run.py
"""

from pathlib import Path

import numpy as np

from k37.sim import api

job = api.load(Path(__file__).with_name("dwell.toml"))
result = api.run(job)
report = result.report
print(f"{job.name}: {report['status']}, {report['cycles']:,} cycles, contour error max "
      f"{report['path']['max_contour_error']:.2f} LSB")

# The traces: one numpy array per CSV column, one value per sample (every 1000 cycles).
t = result.traces["cycle"] / report["clock_hz"]
following = np.abs(result.traces["x_error"])
print(f"largest X following error {following.max():.0f} LSB at {t[following.argmax()]:.3f} s")
for block in report["blocks"]:
    print(f"  N{block['line']} {block['kind']}: cycles {block['start_cycle']:,} to "
          f"{block['end_cycle']:,}, {block['fp_pulses']} FP")

assert report["status"] == "ok" and report["end_point"]["reached"]
assert following.max() <= report["axes"]["x"]["max_abs_error"]

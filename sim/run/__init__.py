"""Running a job: the firmware on the simulated machine or over a link, sampling, measuring,
the report and its outputs."""

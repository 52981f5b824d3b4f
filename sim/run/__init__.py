"""Running a job: the 8085 link, sampling, the report and its outputs."""

"""The two verdicts of a run, STABLE and SAFE, on any run's series: a bag of a simulated or a real session
(``bag_series``) or the in-process runner's result (docs/EXPERIMENTS.md, "The run verdict"). Pure numpy, no
simulator: a hardware session is judged with this package alone."""

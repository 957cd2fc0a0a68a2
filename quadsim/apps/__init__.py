"""Applications: the command line, headless runs, the benchmark, evaluation, re-simulation and exports."""

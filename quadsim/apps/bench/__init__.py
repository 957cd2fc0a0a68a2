"""The benchmark behind `quadsim bench`, a section per module: each figure as a rate and as a
ratio against a baseline measured in the same run (the machines are shared and noisy, so only
ratios taken together mean something). `bench --section NAME` runs one (`sections.RUNS`), in the
order `all` runs them."""

"""Sweeps: the product of scenarios, controllers, airframes, wind settings and seeds, each a
headless run measured with flight metrics, run on a process pool or Ray, gathered in one table.

spec.py reads the sweep file into runs; run.py flies one run (a pure function of its spec);
backends.py runs many on a pool or Ray; table.py keeps the results; report.py summarises and
plots them.
"""

"""Monte Carlo sweeps: axes, expansion into chunks, executors (local, Ray), the resumable store,
aggregation and the report.
"""

#: Where a sweep can run (here, so that the command line's parser reads them without importing
#: the executors).
EXECUTORS = ("local", "ray")

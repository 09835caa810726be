"""The loops that run the stages: the closed FCW loop (truth → sensors → filters → fusion →
warning → metrics, the driver reacting) and the open estimation loop.
"""

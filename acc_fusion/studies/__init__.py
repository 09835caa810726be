"""Studies built on the loops: method comparisons, conformance, traffic and estimation studies.
Nothing in the library imports them.
"""

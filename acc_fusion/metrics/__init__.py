"""Stage 6, metrics: false alarms, misses, lead time against the oracle, rates with intervals and
the FCW test protocols.
"""

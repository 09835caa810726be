"""Shared foundations of every stage: errors, input validation, config loading, pair slots,
atomic output files and plotting helpers. Imports nothing else from acc_fusion.
"""

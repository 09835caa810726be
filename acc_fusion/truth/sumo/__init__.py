"""SUMO as a truth source: the in-process source (libsumo or TraCI), its background process and
the compiled per-vehicle reader.
"""

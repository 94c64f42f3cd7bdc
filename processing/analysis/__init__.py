"""Burn measurement on a metric mesh: per-view probabilities carried onto the surface, fused, measured."""

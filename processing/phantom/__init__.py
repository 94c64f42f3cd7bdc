"""Burn phantoms: rendered multi-view photo sets of a body part with a burn of exactly known geometry."""

"""Healing over time: a burn's visits registered to the first one, its healing rate and review prompts."""

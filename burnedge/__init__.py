"""The composition root: the `burnedge` command line and the demo, the only modules that may import every layer."""

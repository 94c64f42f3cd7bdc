"""The burn center's side of store-and-forward (`burnedge central`)."""

"""Burn segmentation: the network, its training data and training, and ONNX inference on the CPU."""

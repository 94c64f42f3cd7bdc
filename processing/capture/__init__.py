"""Capture intake science: decoding phone pictures, the instant quality gate, frames from video."""

"""Capture: a phone's photos and videos into the gateway (resumable tus uploads, the instant verdict on each
picture, frames taken from a video, thumbnails) and the stored assets; the controllers beside their services."""

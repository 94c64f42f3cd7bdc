"""Analyses: asking for a 3D measurement of an encounter's pictures, its progress and result, and the segmentation
model it uses; the controllers beside the service. The queue, the workers and the runner are gateway/jobs/."""

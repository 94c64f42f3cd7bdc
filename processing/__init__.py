"""The science, pure of servers: clinical calculators and decision support, capture checks, reconstruction (SfM and
MVS), segmentation, burn analysis on the 3D surface, the healing track, the PDF report, the FHIR export, views and
phantoms; `stages.py` is the resumable-stage plumbing they share."""

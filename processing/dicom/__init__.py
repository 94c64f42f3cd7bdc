"""An encounter as one DICOM study (docs/dicom.md): photos, measurements, surface and report."""

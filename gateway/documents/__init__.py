"""Documents of an encounter: the clinical PDF report and the FHIR R4 export, each made from the one encounter
snapshot (schemas/encounter_snapshot.py) read by ReportService; their controllers beside their services."""

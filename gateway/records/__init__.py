"""Patients and their records: patients, encounters and the encounter's parts (intake, ABCDE, secondary survey,
mechanism, burn chart, fluids), the checks every write passes, the calculators and decision support run on every
change, and the audit trail; the controllers beside their services."""

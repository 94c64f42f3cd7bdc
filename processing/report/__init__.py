"""The clinical PDF report: its composition, and the drawings (body chart, plots, burn surface) it prints."""

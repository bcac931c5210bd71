"""The studies behind scripts/cosim study (scripts/study.py runs studies.cli.main)."""

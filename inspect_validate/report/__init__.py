"""Presenting results: text tables for the terminal and versioned JSON files."""

from inspect_validate.report.jsonfile import measurement_document, write_json
from inspect_validate.report.tables import format_measurement, render_table

__all__ = ["format_measurement", "measurement_document", "render_table", "write_json"]

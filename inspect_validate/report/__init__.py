"""Presenting results: versioned JSON files, report pages and plots (text tables for the
terminal are :mod:`inspect_validate.text`'s and each result's ``table()``)."""

from inspect_validate.report.jsonfile import measurement_document, write_json

__all__ = ["measurement_document", "write_json"]

"""Shared foundations: errors, validation, array artifacts, progress."""

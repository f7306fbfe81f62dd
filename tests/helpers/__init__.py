"""Importable helpers of the test suite (worker processes import them by name)."""

"""The package version (one place; the store records it with every study)."""

__version__ = "0.1.0"

"""The version of aeroid (one place: the package and the study provenance read it)."""

__version__ = "0.1.0"

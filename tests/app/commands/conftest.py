"""Fixtures of the dataset tests that the ``mcnkit data`` tests use too."""

from tests.datasets.conftest import tiny_houseexpo

__all__ = ["tiny_houseexpo"]

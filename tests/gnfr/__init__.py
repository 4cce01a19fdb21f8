"""Tests of the gnfr package."""

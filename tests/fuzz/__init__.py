"""Hostile inputs, generated (Hypothesis): see ``conftest.py`` for the rule and the profiles."""

"""Executing plans in a world model of the true scene."""

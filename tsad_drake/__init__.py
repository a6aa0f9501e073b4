"""TSAD on Drake."""

"""Hybrid physics/ML modeling of an aluminum electrolysis cell (CoSTA replication)."""

__version__ = "0.1.0"

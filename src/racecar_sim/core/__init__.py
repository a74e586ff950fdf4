"""Core helpers shared by every layer: sim time, seeded randomness, errors."""

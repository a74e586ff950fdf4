"""Core helpers shared by every layer: sim time and its scheduler, seeded randomness, errors, transforms."""

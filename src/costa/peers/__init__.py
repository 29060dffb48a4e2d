"""Discovery against its peers: PySINDy and the UDE recipe on the same cases, scored alike."""

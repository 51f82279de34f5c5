"""Sample clips (placeholder until the data issue lands: see stagger_nb.data.prepare)."""

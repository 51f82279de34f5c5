"""Prepare data/ (placeholder; filled in by the foundation work)."""
if __name__ == "__main__":
    print("stagger_nb.data.prepare: nothing to do yet")

"""Model -> block IR -> Structured Text."""

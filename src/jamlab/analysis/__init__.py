"""Analysis of traces: avalanches, power-law fits, moduli moments (pure functions on arrays)."""

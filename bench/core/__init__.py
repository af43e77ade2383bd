"""Infrastructure every benchmark shares: plans (cells, entries, tuning jobs), the executor,
tuning, scores, statistics, provenance and roles."""

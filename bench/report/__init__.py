"""Generic writers of tables and figures (Markdown/CSV tables, matplotlib figures)."""

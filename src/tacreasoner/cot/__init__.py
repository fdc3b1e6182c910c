"""TouchCoT builder: cues, teacher prompts and backends, filtering, audit and training files (paper §3.1)."""

"""Tasks: property vocabularies, QA item schema, QA builders, answer extraction and scoring."""

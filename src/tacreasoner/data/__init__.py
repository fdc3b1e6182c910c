"""data part of TacReasoner."""

"""sim part of TacReasoner."""

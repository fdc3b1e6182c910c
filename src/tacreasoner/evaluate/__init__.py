"""evaluate part of TacReasoner."""

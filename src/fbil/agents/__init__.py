"""Task-specific agents: TD3 experts (online and offline) that produce demonstrations."""

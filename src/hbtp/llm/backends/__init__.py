"""LLM backends: oracle, noisy oracle, replay/record, OpenAI-compatible servers, a local model."""

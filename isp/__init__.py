"""isp — a RAW processing pipeline, one replaceable operation at a time."""

"""Accuracy and cost: edgeaa against sample-based methods and real rasterizers."""

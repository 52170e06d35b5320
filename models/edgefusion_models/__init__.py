"""EdgeFusion segmentation network: definition, training data, float -> int8 export (docs/model_format.md)."""

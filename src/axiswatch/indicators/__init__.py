"""The product default: physical indicators of an axis, scored in spreads of its own and its fleet."""

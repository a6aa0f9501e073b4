"""The prehensile decision network: its input encoding, model, dataset, training, weights and
its FeasibilityModel (`net`)."""

"""What a reader sees: the customer's report and its templates, and the generator of the docs' figures and tables."""

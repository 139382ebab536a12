"""Training: the shared loop, the window sampler, and what each part learns from."""

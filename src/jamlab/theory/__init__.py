"""Mean-field theory: Parisi functions, the static jump distribution, the exact cascade sampler."""

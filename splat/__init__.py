"""splat — N-channel Gaussian splatting in JAX, trained on RAW images from several cameras."""

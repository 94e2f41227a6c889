"""The paper's method: PCHIP resampling, |STFT| features, PCA or LRA, and HealthModel."""

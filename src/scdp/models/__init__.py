"""Networks: the conditional 1-D U-Net, the scene autoencoder and the style predictor."""

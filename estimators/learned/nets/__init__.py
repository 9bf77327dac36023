"""Plain ``torch.nn.Module`` networks used by the neural inpainters.

Importing this package imports torch; ``import estimators`` alone does not.
"""

from .unet import ConvBlock, UNet, UNetDecoder, UNetEncoder, pad_to_multiple

__all__ = ["ConvBlock", "UNet", "UNetDecoder", "UNetEncoder", "pad_to_multiple"]

"""Image agreement between a render and the photo: RMSE on down-sampled images, SSIM (Wang et al. 2004) and
NVIDIA ꟻLIP (Andersson et al. 2020), all on sRGB values in [0, 1]; and the differentiable pieces of the losses
(luma, area down-sampling)."""

from __future__ import annotations

import cv2
import numpy as np
import torch
import torch.nn.functional as F


def rmse(a: np.ndarray, b: np.ndarray, factor: int = 8) -> float:
    """Root mean squared difference of two [H, W, 3] images after area down-sampling by ``factor`` (the
    paper's RMSE on down-sampled images, which forgives small misalignment)."""
    size = (max(1, a.shape[1] // factor), max(1, a.shape[0] // factor))
    small_a = cv2.resize(np.asarray(a, np.float32), size, interpolation=cv2.INTER_AREA)
    small_b = cv2.resize(np.asarray(b, np.float32), size, interpolation=cv2.INTER_AREA)
    return float(np.sqrt(np.mean((small_a - small_b) ** 2)))


def ssim(a: np.ndarray, b: np.ndarray, sigma: float = 1.5) -> float:
    """Mean structural similarity of the Rec. 709 luma of two [H, W, 3] images in [0, 1] (Gaussian window of
    ``sigma`` pixels, the standard constants K1 = 0.01, K2 = 0.03)."""
    return float(ssim_map(a, b, sigma).mean())


def ssim_map(a: np.ndarray, b: np.ndarray, sigma: float = 1.5) -> np.ndarray:
    """The per-pixel structural similarity index [H, W] that :func:`ssim` averages."""
    weights = np.array([0.2126, 0.7152, 0.0722], np.float64)
    x, y = np.asarray(a, np.float64) @ weights, np.asarray(b, np.float64) @ weights
    c1, c2 = 0.01**2, 0.03**2

    def blur(z: np.ndarray) -> np.ndarray:
        return cv2.GaussianBlur(z, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)

    mx, my = blur(x), blur(y)
    vx, vy, cxy = blur(x * x) - mx * mx, blur(y * y) - my * my, blur(x * y) - mx * my
    return ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2))


def flip(test: np.ndarray, reference: np.ndarray) -> float:
    """Mean ꟻLIP error of ``test`` against ``reference`` ([H, W, 3] sRGB in [0, 1]; LDR, the default 67 pixels
    per degree): 0 for identical images, towards 1 for maximally different ones. Needs no weights."""
    import flip_evaluator

    as32 = lambda x: np.ascontiguousarray(np.clip(x, 0.0, 1.0), dtype=np.float32)  # noqa: E731
    _, mean, _ = flip_evaluator.evaluate(as32(reference), as32(test), "LDR", inputsRGB=True, applyMagma=False)
    return float(mean)


def luminance(rgb: torch.Tensor) -> torch.Tensor:
    """Rec. 709 luma of an [..., 3] image."""
    return rgb @ torch.tensor([0.2126, 0.7152, 0.0722], dtype=rgb.dtype)


def downsampled(rgb: torch.Tensor, factor: int) -> torch.Tensor:
    """An [H, W, C] image area-averaged by ``factor`` (the paper's 1/8 image loss)."""
    return F.avg_pool2d(rgb.permute(2, 0, 1)[None], factor, ceil_mode=True)[0].permute(1, 2, 0)

//! Image-quality and detection metrics: GMS/GMSD, MSE/PSNR, SSIM/MSSIM, miss rate, AP.

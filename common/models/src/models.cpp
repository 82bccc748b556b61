// placeholder translation unit; replaced by the real implementation

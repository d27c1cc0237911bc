"""The drive's and the plant's parameters: their specs, their validation and the presets."""

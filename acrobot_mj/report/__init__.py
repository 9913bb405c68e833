"""What the package shows: figures, MP4 videos and the validation report."""

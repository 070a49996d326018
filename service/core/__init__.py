"""conformorph service/core."""

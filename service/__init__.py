"""conformorph service."""

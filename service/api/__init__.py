"""conformorph service/api."""

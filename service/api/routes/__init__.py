"""conformorph service/api/routes."""

"""service: the FastAPI job service and the operator CLI. Built in the job-service issue."""

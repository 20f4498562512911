"""The REST API's parts: one router per resource (robots, jobs, a job's events), the request
dependencies (tokens, the store, the job manager) and the errors' HTTP statuses. The app itself
is built by `service.app.create_app`."""

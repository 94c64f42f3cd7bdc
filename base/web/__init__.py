"""HTTP plumbing both servers mount: authentication, problem+json errors, health, login and admin controllers."""

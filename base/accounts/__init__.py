"""Accounts, sessions, paired devices, permissions and login throttling, as both servers use them."""

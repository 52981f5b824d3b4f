"""The 8085 host firmware model and the G-code front end."""

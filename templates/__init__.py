"""Jinja2 templates of the generated modules (data; shipped as mountid.templates)."""

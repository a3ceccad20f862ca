# The Python API reference (`make reference`): Sphinx's autodoc over the built module's docstrings
# (pybind11's typed signatures, the same lines the stubs are generated from), with Debian's Sphinx.
import haustra

project = "haustra"
release = version = haustra.__version__
extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon"]
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "undoc-members": True, "show-inheritance": True}
autodoc_typehints = "signature"
html_theme = "alabaster"
html_theme_options = {"page_width": "1100px", "sidebar_width": "230px"}
exclude_patterns = ["_build"]
nitpicky = False

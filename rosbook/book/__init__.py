"""Book-build tooling: building and reading the HTML book (``pages``) and the Sphinx
extension that ships MeshCat's viewer (``sphinx_meshcat``)."""

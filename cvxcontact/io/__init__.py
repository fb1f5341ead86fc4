"""Input and output: scene files and their expression language, VTU/JSON output, figures."""

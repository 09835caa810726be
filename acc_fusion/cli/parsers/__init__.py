"""The parsers of the ``acc-fusion`` commands, one module per command, each with
``add_parser(subparsers, summary)``: light to import, so that ``--help`` and a usage error
answer at once and an output path is checked before the command's own module (its work, in
:mod:`acc_fusion.cli`) is imported."""

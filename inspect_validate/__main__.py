from inspect_validate.cli import main

main()

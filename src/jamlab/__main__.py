from jamlab.cli import main

main()

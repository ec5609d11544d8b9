from .render import main

main()

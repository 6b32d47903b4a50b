from fbil.cli import main

raise SystemExit(main())

"""A virtual IRC5's RAPID task: an interpreter that executes a RAPID program module (the
shipped `ScrewcalServer.mod`, or a cell's adapted copy) with the controller's semantics, on the
AST of `screwcal.rapid`.

    errors       the controller's error numbers, RapidError, the load-time check's LoadError
    values       num (a 32-bit float), string (<= 80 characters), bool, records, arrays
    operator     the FlexPendant (TPWrite, TPReadFK, TPErase) and the event log
    strings      the string and arithmetic functions
    sockets      the socket instructions on real OS sockets
    motion       MoveAbsJ/MoveJ/MoveL, CJointT, CRobT, CalcJointT, onto the emulated world
    interpreter  the task: data, routines, error handlers (RETRY, TRYNEXT, RAISE), UNDO
"""

"""simulators: the IRC5 and measuring-arm emulators around a true robot built from screwcal's
kinematics. Built in the controller-link issue."""

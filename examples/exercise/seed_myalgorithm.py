"""The seed exercise's script template (MyAlgorithm.py) with its own example, as written there:
pick blue_ball with a vertical grasp and place it on blue_target.

    robocell run examples/exercise/seed_myalgorithm.py

``self`` has ``pick_place`` (the API), ``pauseevent`` and ``stopevent`` (set while the algorithm
may run; Ctrl-C clears stopevent).
"""


def myalgorithm(self):
    ############## Insert your code here ###############
    # Move the robot back to home as a start
    self.pick_place.back_to_home()

    # insert following two lines where you want to pause or stop the algorithm
    # with the stop button in GUI
    while (not self.pauseevent.isSet()) or (not self.stopevent.isSet()):
        if not self.stopevent.isSet():
            return

    ##### A brief example to pick and place object "blue_ball" #####
    object_name = "blue_ball"
    # get object pose
    pose = self.pick_place.get_object_pose(object_name)

    # generate grasp message and pick it up
    # parameters WIDTH and LENGTH need to be tuned according to the object and grasping pose
    WIDTH = 0.3
    LENGTH = 0.15
    grasp = self.pick_place.generate_grasp(
        object_name, "vertical", pose.position, WIDTH, length=LENGTH
    )
    self.pick_place.pickup(object_name, [grasp])

    # setup stop signal detector
    while (not self.pauseevent.isSet()) or (not self.stopevent.isSet()):
        if not self.stopevent.isSet():
            return

    # choose target position and place the object
    target_name = "blue_target"
    place_position = self.pick_place.get_target_position(target_name)
    self.pick_place.place("vertical", place_position)

    ####################################################
